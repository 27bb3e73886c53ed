import numpy as np
def q(P):
    a=abs(P[1]-P[2]);b=abs(P[0]-P[2]);c=abs(P[0]-P[1])
    return (b+c-a)*(c+a-b)*(a+b-c)/(a*b*c)
# conformal map f=exp(g z): relative size gradient g per unit length; equilateral side 1
w=np.exp(2j*np.pi*np.arange(3)/3)/np.sqrt(3)
for g in [0.05,0.1,0.2,0.3]:
    ds=[1-q(np.exp(g*(w*np.exp(1j*th))) ) for th in np.linspace(0,2*np.pi,13)]
    print(g, np.mean(ds), np.mean(ds)/g**2)
# B: mean over triangles (density 1/d^2) of |grad d|^2
x=np.linspace(0,1,801); X,Y=np.meshgrid(x,x)
d=0.01+0.2*((X-.5)**2+(Y-.5)**2); g2=(0.4**2)*((X-.5)**2+(Y-.5)**2)
w8=1/d**2; print("B mean |grad d|^2 over tris", (g2*w8).sum()/w8.sum(), "ntri est", w8.mean()/(np.sqrt(3)/4))
x=np.linspace(0,2,1601); y=np.linspace(0,1,801); X,Y=np.meshgrid(x,y)
r=np.minimum(np.hypot(X-.5,Y-.5),np.hypot(X-1.5,Y-.5)); m=r>0.2
d=0.02+0.1*np.maximum(r-0.2,0); g2=np.where(r>0.2,0.01,0)
w8=m/d**2; print("C mean |grad d|^2", (g2*w8).sum()/w8.sum(), "ntri est", w8.sum()*(2/1600/800)/(np.sqrt(3)/4))
