import sys; from mtools import *
from scipy.spatial import cKDTree
z=np.load(sys.argv[1]); p,t=z['p'],z['t']; case=sys.argv[2]
p0,t0=load(engine_mesh(case))
b0=np.unique(boundary_edges(t0)); b=np.unique(boundary_edges(t))
x0,y0,x1,y1=BOX[case]
onbox=lambda P:(np.isclose(P[:,0],x0)|np.isclose(P[:,0],x1)|np.isclose(P[:,1],y0)|np.isclose(P[:,1],y1))
hole=lambda P:np.zeros(len(P),bool) if case=="B" else (np.abs(np.minimum(np.hypot(P[:,0]-.5,P[:,1]-.5),np.hypot(P[:,0]-1.5,P[:,1]-.5))-0.2)<1e-9)
print("boundary nodes orig",len(b0),"now",len(b), "all on box or hole circle:", bool((onbox(p[b])|hole(p[b])).all()))
dd,_=cKDTree(p0[b0][hole(p0[b0])]).query(p[b][hole(p[b])]) if case=="C" else (np.zeros(1),0)
print("hole nodes kept exactly:", hole(p[b]).sum(), "max displacement", dd.max())
corners=np.array([[x0,y0],[x1,y0],[x0,y1],[x1,y1]]); print("corners present:", (cKDTree(p).query(corners)[0]<1e-12).all())
